// LayerLinkCheck.cpp: the stub program each layer's objects are linked into, whole, with only
// the layers below it (src/CMakeLists.txt, nimbus_layer): it links only if no object of the
// layer calls into a higher one. It is never run.
int main()
{
    return 0;
}
